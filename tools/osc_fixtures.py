#!/usr/bin/env python3
"""Writes this project's own OpenSCENARIO fixtures of the standard test cases (stdlib only).

The cases are written from the public test definitions, in this project's own words and layout:
the Euro NCAP AEB Car-to-Car Rear cases (a vehicle under test, VUT, approaching a global vehicle
target, GVT, that stands, CCRs, or brakes, CCRb; 100 % overlap) and a UN R157 Annex 5-style
cut-in (another vehicle changes into the lane of the vehicle under test). They are fixtures for the
importer and the esmini comparison, not the standard suites themselves (those are issue 22).

    python3 tools/osc_fixtures.py          # rewrites the files listed in FILES

Then `python3 tools/esmini_reference.py` regenerates their esmini references.
"""

import pathlib

OUT = pathlib.Path(__file__).resolve().parents[1] / "tests" / "data" / "openscenario"
DATE = "2026-12-01T00:00:00"


class X:
    """A tiny XML element: tag, attributes (in order), children; written with 2-space indents."""

    def __init__(self, tag, *children, **attrs):
        self.tag, self.children, self.attrs = tag, list(children), attrs

    def lines(self, depth=0):
        pad = "  " * depth
        attrs = "".join(f' {k.rstrip("_")}="{v}"' for k, v in self.attrs.items())
        if not self.children:
            return [f"{pad}<{self.tag}{attrs}/>"]
        out = [f"{pad}<{self.tag}{attrs}>"]
        for c in self.children:
            out.extend(c.lines(depth + 1))
        out.append(f"{pad}</{self.tag}>")
        return out


def document(comment, minor, description, *body):
    head = X("FileHeader", revMajor="1", revMinor=str(minor), date=DATE, author="flc", description=description)
    text = "\n".join(X("OpenSCENARIO", head, *body).lines())
    return f'<?xml version="1.0" encoding="UTF-8"?>\n<!-- {comment.strip()}\n-->\n{text}\n'


def params(*decls):
    return X("ParameterDeclarations", *[X("ParameterDeclaration", name=n, parameterType=t, value=v) for n, t, v in decls])


def road(path="roads/straight.xodr"):
    return X("RoadNetwork", X("LogicFile", filepath=path))


def car(name, vehicle):
    """A 4.5 x 1.8 x 1.5 m passenger car, reference point on the rear axle, box centre 1.4 m ahead."""
    return X(
        "ScenarioObject",
        X(
            "Vehicle",
            X("BoundingBox", X("Center", x="1.4", y="0.0", z="0.75"), X("Dimensions", width="1.8", length="4.5", height="1.5")),
            X("Performance", maxSpeed="70.0", maxAcceleration="10.0", maxDeceleration="10.0"),
            X(
                "Axles",
                X("FrontAxle", maxSteering="0.5", wheelDiameter="0.6", trackWidth="1.6", positionX="2.8", positionZ="0.3"),
                X("RearAxle", maxSteering="0.0", wheelDiameter="0.6", trackWidth="1.6", positionX="0.0", positionZ="0.3"),
            ),
            X("Properties"),
            name=vehicle,
            vehicleCategory="car",
        ),
        name=name,
    )


def speed(target, shape="step", dimension="time", value="0.0"):
    return X(
        "PrivateAction",
        X("LongitudinalAction", X("SpeedAction", X("SpeedActionDynamics", dynamicsShape=shape, dynamicsDimension=dimension, value=value),
                                   X("SpeedActionTarget", X("AbsoluteTargetSpeed", value=target)))),
    )


def teleport(lane, s):
    return X("PrivateAction", X("TeleportAction", X("Position", X("LanePosition", roadId="1", laneId=str(lane), offset="0.0", s=s))))


def place(entity, lane, s, v, *more):
    return X("Private", teleport(lane, s), speed(v), *more, entityRef=entity)


def condition(name, inner, edge="none", delay="0"):
    return X("Condition", inner, name=name, delay=delay, conditionEdge=edge)


def after(t, rule="greaterThan"):
    return X("ByValueCondition", X("SimulationTimeCondition", value=t, rule=rule))


def by_entity(entity, inner):
    return X("ByEntityCondition", X("TriggeringEntities", X("EntityRef", entityRef=entity), triggeringEntitiesRule="any"),
             X("EntityCondition", inner))


def trigger(tag, *groups):
    return X(tag, *[X("ConditionGroup", *g) for g in groups])


def event(name, action_name, action, start, priority="override"):
    return X("Event", X("Action", action, name=action_name), trigger("StartTrigger", [start]), name=name, priority=priority,
             maximumExecutionCount="1")


def story(name, act, actor, maneuver, events, act_start=None):
    group = X("ManeuverGroup", X("Actors", X("EntityRef", entityRef=actor), selectTriggeringEntities="false"),
              X("Maneuver", *events, name=maneuver), name=f"{actor}Group", maximumExecutionCount="1")
    act_el = X("Act", group, *( [trigger("StartTrigger", [act_start])] if act_start is not None else []), name=act)
    return X("Story", act_el, name=name)


def storyboard(init, stories, stop_groups):
    return X("Storyboard", X("Init", X("Actions", *init)), *stories, trigger("StopTrigger", *stop_groups))


def ccrs():
    comment = """flc test fixture, written for this project (tools/osc_fixtures.py) after the public Euro NCAP
    AEB Car-to-Car definition of the rear-stationary case: the vehicle under test (VUT) drives at
    TestSpeed_kmh (50) in lane -2 of the straight 3-lane road toward a stationary global vehicle
    target (GVT) StartDistance (100 m between reference points, 95.5 m freespace) ahead, 100 %
    overlap. esmini's default controller does not brake, so the storyboard stops when the freespace
    gap is under 2 m (t = 93.5 / 13.889 = 6.73 s) or at 10 s. OpenSCENARIO 1.0: an Act
    StartTrigger, priority "overwrite" (1.0's name of override), no coordinateSystem. The VUT's
    speed is held by a step SpeedAction at t > 0."""
    vut_hold = event("HoldTestSpeed", "HoldTestSpeedAction", speed("${$TestSpeed_kmh / 3.6}"), condition("AtStart", after("0.0")),
                     priority="overwrite")
    near = by_entity("VUT", X("RelativeDistanceCondition", entityRef="GVT", value="2.0", freespace="true", rule="lessThan",
                                relativeDistanceType="longitudinal"))
    return document(
        comment, 0, "CCRs-like: VUT at 50 km/h toward a stationary target 100 m ahead (OpenSCENARIO 1.0)",
        params(("TestSpeed_kmh", "double", "50.0"), ("StartDistance", "double", "100.0")),
        X("CatalogLocations"), road(),
        X("Entities", car("VUT", "vut"), car("GVT", "gvt")),
        storyboard(
            [place("VUT", -2, "50.0", "${$TestSpeed_kmh / 3.6}"), place("GVT", -2, "${50 + $StartDistance}", "0.0")],
            [story("RearStationary", "Approach", "VUT", "VUTManeuver", [vut_hold], act_start=condition("ActStart", after("0.0")))],
            [[condition("CloseToTarget", near)], [condition("TimeOut", after("10.0"))]],
        ),
    )


def ccrb():
    comment = """flc test fixture, written for this project (tools/osc_fixtures.py) after the public Euro NCAP
    AEB Car-to-Car definition of the rear-braking case: VUT and GVT both at TestSpeed_kmh (50) in
    lane -2, Gap (12 m) freespace apart, 100 % overlap; at t > BrakeTime (2 s) the GVT brakes to a
    stop at Decel (6 m/s2; the protocol's other level is 2) as a linear SpeedAction by rate (the
    protocol's 1 s ramp to the level is not modelled here). esmini's VUT does not react, so it hits
    the GVT about 2.0 s after the brake starts (freespace 12 - 3 tau^2). The storyboard stops on the
    CollisionCondition (VUT with GVT) or at 10 s. OpenSCENARIO 1.1 (priority "overwrite")."""
    brake = event("GVTBrake", "GVTBrakeAction", speed("0.0", "linear", "rate", "$Decel"), condition("BrakeStart", after("$BrakeTime")),
                  priority="overwrite")
    hit = by_entity("VUT", X("CollisionCondition", X("EntityRef", entityRef="GVT")))
    return document(
        comment, 1, "CCRb-like: the target brakes at 6 m/s2 from 50 km/h, 12 m ahead; stop on collision",
        params(("TestSpeed_kmh", "double", "50.0"), ("Gap", "double", "12.0"), ("Decel", "double", "6.0"), ("BrakeTime", "double", "2.0")),
        X("CatalogLocations"), road(),
        X("Entities", car("VUT", "vut"), car("GVT", "gvt")),
        storyboard(
            [place("VUT", -2, "50.0", "${$TestSpeed_kmh / 3.6}"), place("GVT", -2, "${50 + $Gap + 4.5}", "${$TestSpeed_kmh / 3.6}")],
            [story("RearBraking", "Braking", "GVT", "GVTManeuver", [brake], act_start=condition("ActStart", after("0.0")))],
            [[condition("Impact", hit)], [condition("TimeOut", after("10.0"))]],
        ),
    )


def cutin():
    comment = """flc test fixture, written for this project (tools/osc_fixtures.py) after the cut-in case of
    UN R157 Annex 5 (another vehicle changes into the lane of the vehicle under test): the vehicle
    under test (Subject) at SubjectSpeed_kmh (60) in lane -2; Intruder at IntruderSpeed_kmh (50) in
    the left lane -1, StartDistance (45.2 m between reference points) ahead. When the longitudinal
    freespace gap Subject -> Intruder falls below TriggerGap (30 m; 40.7 m at t = 0, closing at
    2.78 m/s: t = 3.85 s) the Intruder moves into the Subject's lane (RelativeTargetLane 0 to the
    Subject), sinusoidal in LaneChangeTime (3 s). It ends about 21.5 m ahead, still slower; esmini's
    Subject does not brake and the run stops at 12 s before they meet."""
    lane_change = X("PrivateAction", X("LateralAction", X("LaneChangeAction",
        X("LaneChangeActionDynamics", dynamicsShape="sinusoidal", dynamicsDimension="time", value="$LaneChangeTime"),
        X("LaneChangeTarget", X("RelativeTargetLane", entityRef="Subject", value="0")))))
    gap = by_entity("Subject", X("RelativeDistanceCondition", entityRef="Intruder", value="$TriggerGap", freespace="true", rule="lessThan",
                                   relativeDistanceType="longitudinal", coordinateSystem="entity"))
    return document(
        comment, 2, "Cut-in: a slower car in the left lane changes in 30 m ahead of the vehicle under test",
        params(("SubjectSpeed_kmh", "double", "60.0"), ("IntruderSpeed_kmh", "double", "50.0"), ("StartDistance", "double", "45.2"),
               ("TriggerGap", "double", "30.0"), ("LaneChangeTime", "double", "3.0")),
        X("CatalogLocations"), road(),
        X("Entities", car("Subject", "subject"), car("Intruder", "intruder")),
        storyboard(
            [place("Subject", -2, "20.0", "${$SubjectSpeed_kmh / 3.6}"),
             place("Intruder", -1, "${20 + $StartDistance}", "${$IntruderSpeed_kmh / 3.6}")],
            [story("CutIn", "ChangeIn", "Intruder", "IntruderManeuver", [event("ChangeIn", "ChangeInAction", lane_change, condition("GapBelow", gap))])],
            [[condition("TimeOut", after("12.0"))]],
        ),
    )


def controllers():
    comment = """flc test controller catalog, written for this project (tools/osc_fixtures.py). Each entry is
    named after an flc controller; its properties carry settings other players ignore (esmini runs
    with its default controller under disable_controllers)."""
    entry = X("Controller", params(("TimeGap", "double", "1.5")),
              X("Properties", X("Property", name="flc.controller", value="robust"), X("Property", name="timeGap", value="$TimeGap")),
              name="flc-robust")
    return document(comment, 2, "flc controllers", X("Catalog", entry, name="flc_controllers"))


def catalogs():
    comment = """flc test fixture, written for this project (tools/osc_fixtures.py): entities from catalogs
    (catalogs/VehicleCatalog.xosc, catalogs/flc_controllers.xosc) on the straight 3-lane road.
      Ego  car with the catalog defaults (4.5 x 1.8 x 1.5 m, box centre 1.4 m ahead of the
           reference point), lane -2, s 20, 20 m/s; ObjectController: the flc_controllers entry
           flc-robust with TimeGap assigned 1.8; an ActivateControllerAction (longitudinal) in Init.
           esmini under disable_controllers ignores both.
      Lead car with Length 5.2, RearOverhang 1.1 (centre 1.5 m ahead, rear end 1.1 m behind the
           reference point) and MaxDeceleration 8, lane -2, s 70.33, 15 m/s.
      Van  van with Length 6.0 (centre 1.9 m ahead), lane -1, s 40, 18 m/s.
      EgoSlow: when the freespace gap Ego -> Lead < 20 m (50.33 - 3.65 - 1.1 = 45.58 m at t = 0,
      closing at 5 m/s: t = 5.116 s) the Ego slows to 15 m/s at 4 m/s2. Stop at 10 s."""

    def ref(catalog, entry, *assign):
        kids = [X("ParameterAssignments", *[X("ParameterAssignment", parameterRef=k, value=v) for k, v in assign])] if assign else []
        return X("CatalogReference", *kids, catalogName=catalog, entryName=entry)

    ego = X("ScenarioObject", ref("VehicleCatalog", "car"), X("ObjectController", ref("flc_controllers", "flc-robust", ("TimeGap", "1.8"))), name="Ego")
    lead = X("ScenarioObject", ref("VehicleCatalog", "car", ("Length", "5.2"), ("RearOverhang", "1.1"), ("MaxDeceleration", "8.0")), name="Lead")
    van = X("ScenarioObject", ref("VehicleCatalog", "van", ("Length", "6.0")), name="Van")
    activate = X("PrivateAction", X("ControllerAction", X("ActivateControllerAction", longitudinal="true", lateral="false")))
    near = by_entity("Ego", X("RelativeDistanceCondition", entityRef="Lead", value="20.0", freespace="true", rule="lessThan",
                                relativeDistanceType="longitudinal", coordinateSystem="entity"))
    slow = event("EgoSlow", "EgoSlowAction", speed("15.0", "linear", "rate", "4.0"), condition("EgoNearLead", near))
    return document(
        comment, 2, "Vehicles and a controller from catalogs, with ParameterAssignments",
        X("CatalogLocations", X("VehicleCatalog", X("Directory", path="catalogs")), X("ControllerCatalog", X("Directory", path="catalogs"))),
        road(), X("Entities", ego, lead, van),
        storyboard(
            [place("Ego", -2, "20.0", "20.0", activate), place("Lead", -2, "70.33", "15.0"), place("Van", -1, "40.0", "18.0")],
            [story("CatalogStory", "CatalogAct", "Ego", "EgoManeuver", [slow])],
            [[condition("TimeOut", after("10.0"))]],
        ),
    )


FILES = {
    "ccrs.xosc": ccrs,
    "ccrb.xosc": ccrb,
    "cutin.xosc": cutin,
    "catalogs.xosc": catalogs,
    "catalogs/flc_controllers.xosc": controllers,
}

if __name__ == "__main__":
    for name, make in FILES.items():
        path = OUT / name
        path.write_text(make())
        print(path.relative_to(OUT.parents[2]))
