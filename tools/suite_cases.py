#!/usr/bin/env python3
"""Writes the standard test suites of `scenario suite` (stdlib only): OpenSCENARIO scenarios,
their ParameterValueDistributions, the road, and each suite's `suite.toml` (cases, sources, pass
criteria).

Every file is this project's own, written from the public protocol texts (docs/standard-suites.md
names the protocol, version and section of each case); no third-party scenario file was used.

    python3 tools/suite_cases.py        # rewrites scenarios/suites/ (then the TOML twins, below)

The TOML twins (`<suite>/twins/*.toml`, one per run) are the importer's own conversion:

    for f in scenarios/suites/*/*-runs.xosc; do
      cargo run --release --bin scenario -- convert "$f" --out "$(dirname "$f")/twins"; done

`python3 tools/suite_cases.py --twins` does both; `--out DIR` writes the suites into DIR instead
(tools/asam_qc.py compares that with the committed files).
"""

import math
import pathlib
import subprocess
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from osc_writer import (X, activate, after, by_entity, car, condition, document, event, gap_below, lane_change, lane_position,  # noqa: E402
                        params, place, place_at, road_network, speed, story, storyboard)

ROOT = pathlib.Path(__file__).resolve().parents[1]
OUT = ROOT / "scenarios" / "suites"
G = 9.81

# The cars (osc_writer.car): 4.5 m long, reference point on the rear axle, box centre 1.4 m
# ahead of it: front bumper 3.65 m ahead of the reference point, rear bumper 0.85 m behind.
FRONT, REAR = 3.65, 0.85
# Lane change of a 1.8 m wide car from the centre of a 3.5 m lane into the next one, sinusoidal
# by time (lateral position y(tau) = 3.5 (1 - cos(pi tau)) / 2, tau = t / T): its inner side
# crosses the lane marking when it has moved 3.5 - 1.75 - 0.9 = 0.85 m, at
# tau = acos(1 - 2 * 0.85 / 3.5) / pi.
INTRUSION_FRACTION = math.acos(1.0 - 2.0 * 0.85 / 3.5) / math.pi

# UN R157 paragraph 5.2.3.3: the minimum following distance is the ALKS speed times the time gap
# of this table (linear in between).
R157_TIME_GAP = [(7.2, 1.0), (10, 1.1), (20, 1.2), (30, 1.3), (40, 1.4), (50, 1.5), (60, 1.6)]


def r157_time_gap(v_kmh):
    pts = R157_TIME_GAP
    if v_kmh <= pts[0][0]:
        return pts[0][1]
    for (v0, t0), (v1, t1) in zip(pts, pts[1:]):
        if v_kmh <= v1:
            return round(t0 + (t1 - t0) * (v_kmh - v0) / (v1 - v0), 6)
    return pts[-1][1]


def road_file():
    return """<?xml version="1.0" encoding="UTF-8"?>
<!-- flc standard-suite road (tools/suite_cases.py): one straight road, 3000 m along +x from the
     origin, three right-hand driving lanes of 3.5 m (ids -1, -2, -3; -1 next to the reference
     line), as a test track's straight or a motorway section. Written for this project from the
     ASAM OpenDRIVE 1.6 schema. -->
<OpenDRIVE>
  <header revMajor="1" revMinor="6" name="flc suite straight" version="1.0" date="2026-12-01"
          north="0" south="0" east="0" west="0"/>
  <road name="straight" length="3000.0" id="1" junction="-1">
    <link/>
    <type s="0.0" type="motorway"/>
    <planView>
      <geometry s="0.0" x="0.0" y="0.0" hdg="0.0" length="3000.0">
        <line/>
      </geometry>
    </planView>
    <elevationProfile/>
    <lateralProfile/>
    <lanes>
      <laneSection s="0.0">
        <center>
          <lane id="0" type="none" level="false">
            <link/>
            <roadMark sOffset="0.0" type="solid" weight="standard" color="standard" width="0.15"/>
          </lane>
        </center>
        <right>
""" + "".join(f"""          <lane id="{k}" type="driving" level="false">
            <link/>
            <width sOffset="0.0" a="3.5" b="0.0" c="0.0" d="0.0"/>
            <roadMark sOffset="0.0" type="{'solid' if k == -3 else 'broken'}" weight="standard" color="standard" width="0.15"/>
          </lane>
""" for k in (-1, -2, -3)) + """        </right>
      </laneSection>
    </lanes>
  </road>
</OpenDRIVE>
"""


ROAD = road_network("../roads/straight.xodr")


def maneuver_story(name, actor, events):
    return story(name, f"{name}Act", actor, f"{actor}Maneuver", events, act_start=condition(f"{name}Start", after("0.0")))


def stops(ego, target, timeout):
    """Stop on the first contact of the ego with the target, when the ego has stood still for 1 s,
    or at `timeout`."""
    hit = by_entity(ego, X("CollisionCondition", X("EntityRef", entityRef=target)))
    still = by_entity(ego, X("StandStillCondition", duration="1.0"))
    return [[condition("Impact", hit)], [condition("EgoStopped", still)], [condition("TimeOut", after(timeout))]]


def scenario_doc(comment, description, decls, entities, init, stories, stop_groups):
    return document(comment, 2, description, params(*decls), X("CatalogLocations"), ROAD,
                    X("Entities", *[car(n, n.lower()) for n in entities]), storyboard(init, stories, stop_groups))


def distribution(comment, description, scenario, singles=None, sets=None):
    """A deterministic ParameterValueDistribution over `scenario`: `singles` = [(name, values)]
    (a DistributionSet each, combined), or `sets` = [[(name, value), ...], ...] (value sets)."""
    if sets is not None:
        dist = X("DeterministicMultiParameterDistribution", X("ValueSetDistribution", *[
            X("ParameterValueSet", *[X("ParameterAssignment", parameterRef=n, value=str(v)) for n, v in s]) for s in sets]))
        body = [dist]
    else:
        body = [X("DeterministicSingleParameterDistribution", X("DistributionSet", *[X("Element", value=str(v)) for v in vals]),
                  parameterName=n) for n, vals in singles]
    root = X("ParameterValueDistribution", X("ScenarioFile", filepath=scenario), X("Deterministic", *body))
    head = X("FileHeader", revMajor="1", revMinor="2", date="2026-12-01T00:00:00", author="flc", description=description)
    text = "\n".join(X("OpenSCENARIO", head, root).lines())
    return f'<?xml version="1.0" encoding="UTF-8"?>\n<!-- {comment.strip()}\n-->\n{text}\n'


# ---------------------------------------------------------------------------------------------
# Euro NCAP AEB Car-to-Car, rear cases.

NCAP = "Euro NCAP Test Protocol - AEB Car-to-Car systems, version 4.3"
NCAP_TTC0 = 4.0  # the test starts at TTC = 4 s (the protocol's T0)


def ccrs():
    comment = f"""flc standard suite ncap-ccr (tools/suite_cases.py), written for this project after the
    public {NCAP}, Car-to-Car Rear stationary (CCRs): the vehicle under test (VUT) drives at
    TestSpeed_kmh in lane -2 of the straight road toward a stationary global vehicle target (GVT),
    100 % overlap. The run starts at the protocol's T0, TTC = 4 s: freespace gap = 4 s x test speed
    (GVT reference point at 50 + 3.65 + gap + 0.85 m). From t = 0 the VUT's controller drives
    (the AEB / following function under test is on throughout). Stop: contact, the VUT standing
    for 1 s, or 12 s."""
    gvt_s = f"${{50 + {FRONT + REAR} + $TTCStart * $TestSpeed_kmh / 3.6}}"
    return scenario_doc(
        comment, "CCRs: the VUT approaches a stationary target from TTC 4 s",
        [("TestSpeed_kmh", "double", "50.0"), ("TTCStart", "double", str(NCAP_TTC0))],
        ["VUT", "GVT"],
        [place("VUT", -2, "50.0", "${$TestSpeed_kmh / 3.6}"), place("GVT", -2, gvt_s, "0.0")],
        [],
        stops("VUT", "GVT", "12.0"),
    )


def ccrm():
    comment = f"""flc standard suite ncap-ccr (tools/suite_cases.py), written for this project after the
    public {NCAP}, Car-to-Car Rear moving (CCRm): the VUT at TestSpeed_kmh approaches a GVT
    driving at TargetSpeed_kmh (20) in the same lane, 100 % overlap, from TTC = 4 s (freespace gap
    = 4 s x the speed difference). The VUT's controller drives from t = 0. Stop: contact or 15 s."""
    gvt_s = f"${{50 + {FRONT + REAR} + $TTCStart * ($TestSpeed_kmh - $TargetSpeed_kmh) / 3.6}}"
    hit = stops("VUT", "GVT", "15.0")
    return scenario_doc(
        comment, "CCRm: the VUT approaches a target at 20 km/h from TTC 4 s",
        [("TestSpeed_kmh", "double", "50.0"), ("TargetSpeed_kmh", "double", "20.0"), ("TTCStart", "double", str(NCAP_TTC0))],
        ["VUT", "GVT"],
        [place("VUT", -2, "50.0", "${$TestSpeed_kmh / 3.6}"), place("GVT", -2, gvt_s, "${$TargetSpeed_kmh / 3.6}")],
        [],
        [hit[0], hit[2]],
    )


def ramp_events(actor, decel, start, ramp, steps=10):
    """The target's deceleration ramped linearly to `decel` over `ramp` s from `start`: `steps`
    linear-by-rate SpeedActions to a stop, each overriding the last, at the mean deceleration of
    its slice of the ramp (a staircase whose speed follows the linear ramp's to within
    decel * (ramp / steps)^2 / 8), then the full deceleration."""
    out = []
    for k in range(steps + 1):
        frac = (k + 0.5) / steps if k < steps else 1.0
        t = f"${{{start} + {ramp} * {k / steps}}}"
        rate = f"${{{decel} * {frac}}}"
        out.append(event(f"{actor}Brake{k}", f"{actor}Brake{k}Action", speed("0.0", "linear", "rate", rate),
                         condition(f"{actor}Brake{k}Start", after(t))))
    return out


def ccrb():
    comment = f"""flc standard suite ncap-ccr (tools/suite_cases.py), written for this project after the
    public {NCAP}, Car-to-Car Rear braking (CCRb): VUT and GVT both at TestSpeed_kmh (50) in lane
    -2, Headway (12 or 40 m) freespace apart, 100 % overlap. The VUT is held at the test speed
    and headway by the story (as the test driver / robot does) until the GVT brakes at BrakeTime
    (2 s); then its controller drives. The GVT's deceleration (Decel, 2 or 6 m/s2) is reached
    within RampTime (1 s) after the protocol, here a linear ramp (ramp_events). Stop: contact,
    the VUT standing for 1 s, or 15 s."""
    hand_over = event("HandOver", "HandOverAction", activate("true"), condition("AtBrake", after("$BrakeTime")))
    return scenario_doc(
        comment, "CCRb: the target ahead brakes from 50 km/h, the VUT's controller takes over at the brake onset",
        [("TestSpeed_kmh", "double", "50.0"), ("Headway", "double", "12.0"), ("Decel", "double", "6.0"),
         ("BrakeTime", "double", "2.0"), ("RampTime", "double", "1.0")],
        ["VUT", "GVT"],
        [place("VUT", -2, "50.0", "${$TestSpeed_kmh / 3.6}", activate("false")),
         place("GVT", -2, f"${{50 + {FRONT + REAR} + $Headway}}", "${$TestSpeed_kmh / 3.6}")],
        [maneuver_story("TargetBrake", "GVT", ramp_events("GVT", "$Decel", "$BrakeTime", "$RampTime")),
         maneuver_story("VUTHandOver", "VUT", [hand_over])],
        stops("VUT", "GVT", "15.0"),
    )


# ---------------------------------------------------------------------------------------------
# Euro NCAP 2026 Frontal Collisions, Car-to-Car Rear: the grid of the 2026 rating calculator
# (euroncap-rating-2026, its "FC - Car & PTW pred." sheet): every VUT speed at seven impact
# locations.

NCAP26 = "Euro NCAP 2026 Crash Avoidance - Frontal Collisions (AEB Car-to-Car Rear), grid of the 2026 rating calculator"
# Impact locations, % of the VUT's width, the calculator's columns (the outer two: its extended range).
IMPACT_LOCATIONS = [125, 100, 75, 50, 25, 0, -25]
# ASSUMPTION (the protocol text was not found): the impact location is where the target's
# centreline meets the VUT's front, measured across the VUT's width from its right edge (0 %) to
# its left edge (100 %); 50 % is centred (100 % overlap), 75 / 25 % overlap 75 % on the left /
# right, 100 / 0 % overlap 50 %, 125 / -25 % overlap 25 %. The target's lateral offset from the
# VUT's centreline is (ImpactLocation - 50) / 100 x VUT width (+ left); the sign is this
# parameter (-1 puts 0 % on the left edge instead).
IMPACT_LOCATION_SIGN = 1
VUT_WIDTH = 1.8  # osc_writer.car
CCRS26_SPEEDS = list(range(10, 81, 10))
CCRM26_SPEEDS = [(v, 20) for v in range(30, 81, 10)] + [(90, 30), (100, 40), (110, 50), (120, 60), (130, 70)]
CCRB26_SPEEDS = list(range(30, 131, 10))
# ASSUMPTION (the 2026 protocol's CCRb headway and deceleration were not found in public text):
# the target brakes at 4 m/s2 (reached within 1 s) from 12 m headway at every speed. Both are
# parameters of ccrb.xosc (Headway, Decel); change them here and rewrite the suite.
CCRB26_HEADWAY_M = 12.0
CCRB26_DECEL = 4.0


def gvt_offset():
    return f"${{{IMPACT_LOCATION_SIGN} * ($ImpactLocation - 50) / 100 * {VUT_WIDTH}}}"


def ccrs26():
    comment = f"""flc standard suite ncap-ccr-2026 (tools/suite_cases.py), written for this project after the
    {NCAP26}, CCRs: the VUT at TestSpeed_kmh in lane -2 toward a stationary GVT from TTC = 4 s
    (freespace gap = 4 s x test speed), the GVT's centreline at ImpactLocation % of the VUT's
    width (50 centred; its lateral offset (ImpactLocation - 50) / 100 x {VUT_WIDTH} m, + left: an
    assumption, docs/standard-suites.md). The VUT's controller drives from t = 0. Stop: contact,
    the VUT standing for 1 s, or 12 s."""
    gvt_s = f"${{50 + {FRONT + REAR} + $TTCStart * $TestSpeed_kmh / 3.6}}"
    return scenario_doc(
        comment, "CCRs 2026: the VUT approaches a stationary target at an impact location from TTC 4 s",
        [("TestSpeed_kmh", "double", "50.0"), ("ImpactLocation", "double", "50.0"), ("TTCStart", "double", str(NCAP_TTC0))],
        ["VUT", "GVT"],
        [place("VUT", -2, "50.0", "${$TestSpeed_kmh / 3.6}"), place_at("GVT", lane_position(-2, gvt_s, gvt_offset()), "0.0")],
        [],
        stops("VUT", "GVT", "12.0"),
    )


def ccrm26():
    comment = f"""flc standard suite ncap-ccr-2026 (tools/suite_cases.py), written for this project after the
    {NCAP26}, CCRm: the VUT at TestSpeed_kmh approaches a GVT driving at TargetSpeed_kmh in the
    same lane from TTC = 4 s (freespace gap = 4 s x the speed difference), the GVT's centreline at
    ImpactLocation % of the VUT's width (as in ccrs.xosc). The VUT's controller drives from t = 0.
    Stop: contact or 15 s."""
    gvt_s = f"${{50 + {FRONT + REAR} + $TTCStart * ($TestSpeed_kmh - $TargetSpeed_kmh) / 3.6}}"
    hit = stops("VUT", "GVT", "15.0")
    return scenario_doc(
        comment, "CCRm 2026: the VUT approaches a slower target at an impact location from TTC 4 s",
        [("TestSpeed_kmh", "double", "50.0"), ("TargetSpeed_kmh", "double", "20.0"), ("ImpactLocation", "double", "50.0"),
         ("TTCStart", "double", str(NCAP_TTC0))],
        ["VUT", "GVT"],
        [place("VUT", -2, "50.0", "${$TestSpeed_kmh / 3.6}"),
         place_at("GVT", lane_position(-2, gvt_s, gvt_offset()), "${$TargetSpeed_kmh / 3.6}")],
        [],
        [hit[0], hit[2]],
    )


def ccrb26():
    comment = f"""flc standard suite ncap-ccr-2026 (tools/suite_cases.py), written for this project after the
    {NCAP26}, CCRb: VUT and GVT both at TestSpeed_kmh in lane -2, Headway ({CCRB26_HEADWAY_M:g} m)
    freespace apart, the GVT's centreline at ImpactLocation % of the VUT's width (as in ccrs.xosc).
    The VUT is held at the test speed and headway by the story until the GVT brakes at BrakeTime
    (2 s); then its controller drives. The GVT's deceleration (Decel, {CCRB26_DECEL:g} m/s2) is
    reached within RampTime (1 s), a linear ramp (ramp_events). Headway and Decel are assumptions
    (docs/standard-suites.md). Stop: contact, the VUT standing for 1 s, or 20 s."""
    hand_over = event("HandOver", "HandOverAction", activate("true"), condition("AtBrake", after("$BrakeTime")))
    return scenario_doc(
        comment, "CCRb 2026: the target ahead brakes, the VUT's controller takes over at the brake onset",
        [("TestSpeed_kmh", "double", "50.0"), ("ImpactLocation", "double", "50.0"), ("Headway", "double", str(CCRB26_HEADWAY_M)),
         ("Decel", "double", str(CCRB26_DECEL)), ("BrakeTime", "double", "2.0"), ("RampTime", "double", "1.0")],
        ["VUT", "GVT"],
        [place("VUT", -2, "50.0", "${$TestSpeed_kmh / 3.6}", activate("false")),
         place_at("GVT", lane_position(-2, f"${{50 + {FRONT + REAR} + $Headway}}", gvt_offset()), "${$TestSpeed_kmh / 3.6}")],
        [maneuver_story("TargetBrake", "GVT", ramp_events("GVT", "$Decel", "$BrakeTime", "$RampTime")),
         maneuver_story("VUTHandOver", "VUT", [hand_over])],
        stops("VUT", "GVT", "20.0"),
    )


# ---------------------------------------------------------------------------------------------
# UN R157 (ALKS), Annex 5 test scenarios.

R157 = "UN Regulation No. 157 (ALKS), Annex 5"


def follow_comfortable():
    comment = f"""flc standard suite r157 (tools/suite_cases.py), written for this project after {R157},
    test 4.3 (following a lead vehicle), case 4.3_1: the ALKS vehicle (Ego) follows a lead vehicle
    at EgoSpeed_kmh (60) at the minimum following distance of paragraph 5.2.3.3 (TimeGap 1.6 s x
    speed); at 5 s the lead slows down comfortably (LeadDecel, 1 or 2 m/s2) to LeadEndSpeed_kmh,
    holds it for 10 s and speeds up again at 1 m/s2 to the start speed. The Ego's controller
    drives throughout. Stop: contact or 40 s."""
    lead_s = f"${{50 + {FRONT + REAR} + $TimeGap * $EgoSpeed_kmh / 3.6}}"
    slow = event("LeadSlows", "LeadSlowsAction", speed("${$LeadEndSpeed_kmh / 3.6}", "linear", "rate", "$LeadDecel"),
                 condition("SlowStart", after("5.0")))
    back = event("LeadSpeedsUp", "LeadSpeedsUpAction", speed("${$EgoSpeed_kmh / 3.6}", "linear", "rate", "1.0"),
                 condition("BackStart", after("${5.0 + ($EgoSpeed_kmh - $LeadEndSpeed_kmh) / 3.6 / $LeadDecel + 10.0}")))
    hit = stops("Ego", "Lead", "40.0")
    return scenario_doc(
        comment, "R157 4.3_1: follow a lead that slows down and speeds up comfortably",
        [("EgoSpeed_kmh", "double", "60.0"), ("TimeGap", "double", "1.6"), ("LeadDecel", "double", "2.0"),
         ("LeadEndSpeed_kmh", "double", "30.0")],
        ["Ego", "Lead"],
        [place("Ego", -2, "50.0", "${$EgoSpeed_kmh / 3.6}"), place("Lead", -2, lead_s, "${$EgoSpeed_kmh / 3.6}")],
        [maneuver_story("LeadSpeeds", "Lead", [slow, back])],
        [hit[0], hit[2]],
    )


def follow_emergency():
    comment = f"""flc standard suite r157 (tools/suite_cases.py), written for this project after {R157},
    test 4.3, case 4.3_2 (lead vehicle emergency brake): Ego and lead at EgoSpeed_kmh, the Ego at
    the minimum following distance of paragraph 5.2.3.3 (TimeGap x speed). The Ego is held there
    by the story until the lead brakes to a stop at 2 s at LeadDecel (6 m/s2, the deceleration
    paragraph 5.2.3.4 asks the ALKS to handle); then its controller drives. Stop: contact, the
    Ego standing for 1 s, or 20 s."""
    lead_s = f"${{50 + {FRONT + REAR} + $TimeGap * $EgoSpeed_kmh / 3.6}}"
    brake = event("LeadBrakes", "LeadBrakesAction", speed("0.0", "linear", "rate", "$LeadDecel"), condition("BrakeStart", after("2.0")))
    hand_over = event("HandOver", "HandOverAction", activate("true"), condition("AtBrake", after("2.0")))
    return scenario_doc(
        comment, "R157 4.3_2: the lead ahead brakes to a stop at 6 m/s2",
        [("EgoSpeed_kmh", "double", "60.0"), ("TimeGap", "double", "1.6"), ("LeadDecel", "double", "6.0")],
        ["Ego", "Lead"],
        [place("Ego", -2, "50.0", "${$EgoSpeed_kmh / 3.6}", activate("false")), place("Lead", -2, lead_s, "${$EgoSpeed_kmh / 3.6}")],
        [maneuver_story("LeadBrake", "Lead", [brake]), maneuver_story("EgoHandOver", "Ego", [hand_over])],
        stops("Ego", "Lead", "20.0"),
    )


def cut_in():
    comment = f"""flc standard suite r157 (tools/suite_cases.py), written for this project after {R157},
    test 4.4 (lane change of another vehicle into the lane), case 4.4_1 (cut-in, no collision):
    the Ego at EgoSpeed_kmh (60) in lane -2, a slower Intruder at IntruderSpeed_kmh in lane -1
    ahead. The Intruder changes into the Ego's lane (sinusoidal, LaneChangeTime) when the
    longitudinal freespace gap falls below the one that gives, at the moment its side crosses the
    lane marking (INTRUSION_FRACTION = {INTRUSION_FRACTION:.4f} of the lane change), the time to
    collision of paragraph 5.2.5.2 (v_rel / (2 x 6 m/s2) + 0.35 s) plus Margin (0.5 s): a
    collision the ALKS shall avoid. Its lateral movement is then visible for
    {INTRUSION_FRACTION:.4f} x LaneChangeTime >= 0.72 s before the intrusion (5.2.5.2 (b)) for
    LaneChangeTime >= 2.2 s. The Ego is held at its speed by the story until the lane change
    starts; then its controller drives. Stop: contact or 20 s."""
    vrel = "(($EgoSpeed_kmh - $IntruderSpeed_kmh) / 3.6)"
    trigger_gap = f"${{{vrel} * ({INTRUSION_FRACTION:.6f} * $LaneChangeTime + {vrel} / 12.0 + 0.35 + $Margin)}}"
    start_s = f"${{50 + {FRONT + REAR} + {vrel} * ({INTRUSION_FRACTION:.6f} * $LaneChangeTime + {vrel} / 12.0 + 0.35 + $Margin + 1.0)}}"
    gap = gap_below("Ego", "Intruder", trigger_gap)
    change = event("ChangeIn", "ChangeInAction", lane_change("Ego", "0"), condition("GapBelow", gap))
    hand_over = event("HandOver", "HandOverAction", activate("true"), condition("GapBelowToo", gap))
    hit = stops("Ego", "Intruder", "20.0")
    return scenario_doc(
        comment, "R157 4.4_1: a slower car cuts in at the regulation's time to collision plus 0.5 s",
        [("EgoSpeed_kmh", "double", "60.0"), ("IntruderSpeed_kmh", "double", "40.0"), ("LaneChangeTime", "double", "3.0"),
         ("Margin", "double", "0.5")],
        ["Ego", "Intruder"],
        [place("Ego", -2, "50.0", "${$EgoSpeed_kmh / 3.6}", activate("false")),
         place("Intruder", -1, start_s, "${$IntruderSpeed_kmh / 3.6}")],
        [maneuver_story("CutIn", "Intruder", [change]), maneuver_story("EgoHandOver", "Ego", [hand_over])],
        [hit[0], hit[2]],
    )


def cut_out():
    comment = f"""flc standard suite r157 (tools/suite_cases.py), written for this project after {R157},
    test 4.5 (lane change of the lead vehicle out of the lane), case 4.5_1 (cut-out revealing a
    fully blocking stationary vehicle): the Ego follows a Lead at EgoSpeed_kmh at the minimum
    following distance of paragraph 5.2.3.3 (TimeGap x speed); a stationary Blocker stands in the
    lane 200 m ahead of the lead. When the lead's freespace gap to the Blocker falls below CutOutGap
    the lead changes into the left lane (sinusoidal, LaneChangeTime 3 s) and reveals it. The Ego
    is held at its speed and distance by the story until the lead starts the lane change; then
    its controller drives. Stop: contact with the Blocker, the Ego standing for 1 s, or 30 s."""
    lead_s = f"${{50 + {FRONT + REAR} + $TimeGap * $EgoSpeed_kmh / 3.6}}"
    blocker_s = f"${{50 + {FRONT + REAR} + $TimeGap * $EgoSpeed_kmh / 3.6 + {FRONT + REAR} + 200.0}}"
    near = gap_below("Lead", "Blocker", "$CutOutGap")
    change = event("CutOut", "CutOutAction", lane_change("Lead", "1"), condition("NearBlocker", near))
    hand_over = event("HandOver", "HandOverAction", activate("true"), condition("NearBlockerToo", near))
    return scenario_doc(
        comment, "R157 4.5_1: the lead changes lane and reveals a stationary car",
        [("EgoSpeed_kmh", "double", "60.0"), ("TimeGap", "double", "1.6"), ("CutOutGap", "double", "50.0"),
         ("LaneChangeTime", "double", "3.0")],
        ["Ego", "Lead", "Blocker"],
        [place("Ego", -2, "50.0", "${$EgoSpeed_kmh / 3.6}", activate("false")), place("Lead", -2, lead_s, "${$EgoSpeed_kmh / 3.6}"),
         place("Blocker", -2, blocker_s, "0.0")],
        [maneuver_story("LeadCutOut", "Lead", [change]), maneuver_story("EgoHandOver", "Ego", [hand_over])],
        stops("Ego", "Blocker", "30.0"),
    )


def suite_toml(name, title, source, cases):
    lines = [f'# The {name} suite of `scenario suite` (written by tools/suite_cases.py; docs/standard-suites.md).',
             f'name = "{name}"', f'title = "{title}"', f'source = "{source}"', "",
             "# The vehicle under test keeps its lane: the importer's default for OpenSCENARIO files",
             "# (docs/sim-model.md, \"Steering\").", ""]
    for c in cases:
        lines += ["[[cases]]"] + [f"{k} = {v!r}".replace("'", '"') if not isinstance(v, bool) else f"{k} = {str(v).lower()}"
                                  for k, v in c.items()] + [""]
    return "\n".join(lines)


SUITES = {
    "ncap-ccr": dict(
        title="Euro NCAP AEB Car-to-Car Rear",
        source=NCAP,
        files={"ccrs.xosc": ccrs, "ccrm.xosc": ccrm, "ccrb.xosc": ccrb},
        dists={
            "ccrs-runs.xosc": ("ccrs.xosc", dict(singles=[("TestSpeed_kmh", list(range(10, 81, 5)))]),
                               "CCRs: VUT 10-80 km/h in 5 km/h steps"),
            "ccrm-runs.xosc": ("ccrm.xosc", dict(singles=[("TestSpeed_kmh", list(range(30, 81, 5)))]),
                               "CCRm: VUT 30-80 km/h in 5 km/h steps, target 20 km/h"),
            "ccrb-runs.xosc": ("ccrb.xosc", dict(singles=[("Headway", [12, 40]), ("Decel", [2, 6])]),
                               "CCRb: headway 12 and 40 m, target deceleration 2 and 6 m/s2"),
        },
        cases=[
            dict(id="CCRs", file="ccrs-runs.xosc", ego="VUT", section="Test scenarios: CCRs (stationary target, 10-80 km/h, 100 % overlap)",
                 criterion="ncap"),
            dict(id="CCRm", file="ccrm-runs.xosc", ego="VUT", section="Test scenarios: CCRm (target at 20 km/h, VUT 30-80 km/h, 100 % overlap)",
                 criterion="ncap"),
            dict(id="CCRb", file="ccrb-runs.xosc", ego="VUT",
                 section="Test scenarios: CCRb (both 50 km/h, 12 / 40 m, target braking 2 / 6 m/s2 reached within 1 s)", criterion="ncap"),
        ],
    ),
    "ncap-ccr-2026": dict(
        title="Euro NCAP 2026 AEB Car-to-Car Rear (the rating calculator's grid)",
        source=NCAP26,
        files={"ccrs.xosc": ccrs26, "ccrm.xosc": ccrm26, "ccrb.xosc": ccrb26},
        dists={
            "ccrs-runs.xosc": ("ccrs.xosc", dict(sets=[[("TestSpeed_kmh", v), ("ImpactLocation", il)] for v in CCRS26_SPEEDS
                                                       for il in IMPACT_LOCATIONS]),
                               "CCRs: VUT 10-80 km/h in 10 km/h steps, impact locations 125 to -25 %"),
            "ccrm-runs.xosc": ("ccrm.xosc", dict(sets=[[("TestSpeed_kmh", v), ("TargetSpeed_kmh", g), ("ImpactLocation", il)]
                                                       for v, g in CCRM26_SPEEDS for il in IMPACT_LOCATIONS]),
                               "CCRm: VUT 30-80 km/h behind a target at 20 km/h, 90/30 to 130/70 km/h, impact locations 125 to -25 %"),
            "ccrb-runs.xosc": ("ccrb.xosc", dict(sets=[[("TestSpeed_kmh", v), ("ImpactLocation", il)] for v in CCRB26_SPEEDS
                                                       for il in IMPACT_LOCATIONS]),
                               "CCRb: both 30-130 km/h in 10 km/h steps, impact locations 125 to -25 %"),
        },
        cases=[
            dict(id="CCRs", file="ccrs-runs.xosc", ego="VUT",
                 section="CCRs: stationary target, VUT 10-80 km/h, impact locations 125 to -25 % (outer two: extended range)",
                 criterion="ncap_2026"),
            dict(id="CCRm", file="ccrm-runs.xosc", ego="VUT",
                 section="CCRm: target 20 km/h at VUT 30-80 km/h, then 90/30 to 130/70 km/h, impact locations 125 to -25 %",
                 criterion="ncap_2026"),
            dict(id="CCRb", file="ccrb-runs.xosc", ego="VUT",
                 section=f"CCRb: both 30-130 km/h, {CCRB26_HEADWAY_M:g} m headway, target braking {CCRB26_DECEL:g} m/s2 within 1 s "
                         "(assumed), impact locations 125 to -25 %", criterion="ncap_2026"),
        ],
    ),
    "r157": dict(
        title="UN R157 ALKS, Annex 5 longitudinal scenarios",
        source=R157,
        files={"r157-4.3_1.xosc": follow_comfortable, "r157-4.3_2.xosc": follow_emergency, "r157-4.4_1.xosc": cut_in,
               "r157-4.5_1.xosc": cut_out},
        dists={
            "r157-4.3_1-runs.xosc": ("r157-4.3_1.xosc", dict(singles=[("LeadDecel", [1, 2]), ("LeadEndSpeed_kmh", [20, 30, 40])]),
                                     "4.3_1: lead slows at 1 and 2 m/s2 to 20, 30, 40 km/h"),
            "r157-4.3_2-runs.xosc": ("r157-4.3_2.xosc", dict(sets=[[("EgoSpeed_kmh", v), ("TimeGap", r157_time_gap(v))] for v in (20, 30, 40, 50, 60)]),
                                     "4.3_2: 20-60 km/h, each at its minimum following distance"),
            "r157-4.4_1-runs.xosc": ("r157-4.4_1.xosc", dict(singles=[("IntruderSpeed_kmh", [30, 40, 50]), ("LaneChangeTime", [3, 4])]),
                                     "4.4_1: intruder at 30, 40, 50 km/h, lane change in 3 and 4 s"),
            "r157-4.5_1-runs.xosc": ("r157-4.5_1.xosc", dict(sets=[[("EgoSpeed_kmh", v), ("TimeGap", r157_time_gap(v)), ("CutOutGap", g)]
                                                                   for v in (40, 60) for g in (50, 70)]),
                                     "4.5_1: 40 and 60 km/h, cut-out 50 and 70 m before the stationary car"),
        },
        cases=[
            dict(id="4.3_1", file="r157-4.3_1-runs.xosc", ego="Ego", section="4.3 following a lead vehicle; 4.3_1 comfortable",
                 criterion="no_collision", max_decel=3.5),
            dict(id="4.3_2", file="r157-4.3_2-runs.xosc", ego="Ego", section="4.3 following a lead vehicle; 4.3_2 lead emergency brake (5.2.3.3, 5.2.3.4)",
                 criterion="no_collision"),
            dict(id="4.4_1", file="r157-4.4_1-runs.xosc", ego="Ego", section="4.4 lane change into the lane; 4.4_1 cut-in, no collision (5.2.5.2)",
                 criterion="no_collision"),
            dict(id="4.5_1", file="r157-4.5_1-runs.xosc", ego="Ego", section="4.5 lane change out of the lane; 4.5_1 fully blocking stationary vehicle",
                 criterion="no_collision"),
        ],
    ),
}


def main():
    global OUT
    if "--out" in sys.argv:
        OUT = pathlib.Path(sys.argv[sys.argv.index("--out") + 1]).resolve()
        if "--twins" in sys.argv:
            sys.exit("error: --twins rewrites the committed twins; it does not go with --out")
    (OUT / "roads").mkdir(parents=True, exist_ok=True)
    (OUT / "roads" / "straight.xodr").write_text(road_file())
    written = []
    for name, s in SUITES.items():
        d = OUT / name
        d.mkdir(parents=True, exist_ok=True)
        for f, make in s["files"].items():
            (d / f).write_text(make())
        for f, (scen, kw, desc) in s["dists"].items():
            comment = f"flc standard suite {name} (tools/suite_cases.py): the runs of {scen}; {desc}."
            (d / f).write_text(distribution(comment, desc, scen, **kw))
            written.append(d / f)
        (d / "suite.toml").write_text(suite_toml(name, s["title"], s["source"], s["cases"]))
    if "--twins" in sys.argv:
        for f in written:
            twins = f.parent / "twins"
            for old in twins.glob(f"{f.name.removesuffix('-runs.xosc')}-*.toml"):
                old.unlink()
            subprocess.run(["cargo", "run", "--quiet", "--release", "--bin", "scenario", "--", "convert", str(f), "--out", str(twins)],
                           cwd=ROOT, check=True)
    print("\n".join(str(p.relative_to(OUT.parent)) for p in sorted(OUT.rglob("*.xosc"))))


if __name__ == "__main__":
    main()
