#!/usr/bin/env python3
"""A small OpenSCENARIO XML writer (stdlib only): elements, the document frame and the few actions,
conditions and storyboard pieces the standard suites use. `tools/suite_cases.py` writes the suites
with it; it is not a runnable tool itself.
"""

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
